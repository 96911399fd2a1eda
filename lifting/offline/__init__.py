"""What runs apart from a lift: training and distilling priors, evaluation, benchmarks."""
