"""The motion prior: the network and its checkpoint, its features, the noise schedule, where it runs."""
