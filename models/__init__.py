"""The bundled models: one TOML scene per reference case (package data of ``vibdyn.models``; list them with
``vibdyn.bundled_models()``, load one by name with ``vibdyn.load_scene("four_bar")``)."""
