"""The camera from the scene's straight lines: roll, pitch and (where two orthogonal horizontal directions are seen)
focal length of one static view, from a few grey frames (:func:`estimate.scene_camera`)."""
