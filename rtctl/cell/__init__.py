"""The cell: several robots' daemons coordinated over Zenoh (docs/cell.md)."""
