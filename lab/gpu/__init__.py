"""The gpu studies and reports."""
