"""The guided sampler (the paper's Algorithm 1) and everything it calls per diffusion step."""
