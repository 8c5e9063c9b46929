"""svtrain: the single-image SVBRDF capture network, its training, evaluation and prediction."""
