"""Layer 5, studies: many analyses at once (parameter sweeps on executors or Dask) and example scene builders."""
