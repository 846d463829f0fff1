from runtime_helpers import daemon, write_config  # noqa: F401  (fixtures)
