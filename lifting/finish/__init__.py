"""What happens to a take after sampling: steady depth, rigid people, the one answer, the estimated world."""
