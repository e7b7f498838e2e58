"""ilpss: Incremental Learning of Policy Space Structure: kernels, options, SMDP learning, the lifelong loop, experiments."""
