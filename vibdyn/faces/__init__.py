"""Layer 7, faces: what people touch: the command line (cli), matplotlib plots, the meshcat viewer."""
