"""Reading and writing files safely: atomic writes, bounded reads, npz headers checked before loading."""
