"""What training's studies and fits share: the real HDRs, the folds, the studies' command line and output."""
