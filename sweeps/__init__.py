"""Sweep files shipped with hertzian (the paper's figure groups, examples); TOML data only."""
