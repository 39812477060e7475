"""dpc training: torch PointFilter op, cascade, loss language, trainer, export (docs/training.md)."""
