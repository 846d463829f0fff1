"""Benchmarks that `rtctl bench …` runs on the user's machine: each returns a JSON-able dict and has a
``format_table``; timing goals live here, never in tests."""
