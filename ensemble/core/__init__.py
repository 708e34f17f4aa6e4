"""The core: scene → model → state → solver, and the runner that records an ensemble's run."""
