"""Training: config, batches from the compiled cache, the loop, checkpoints."""
