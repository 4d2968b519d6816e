"""Layer 6, input and output: TOML scene files (scenefile) and robots from URDF, MJCF and example-robot-data
(robots)."""
