"""The learned estimator: its network, losses, training data (Eq. 5 relighting), training, shipping, ablation and cross-validation."""
