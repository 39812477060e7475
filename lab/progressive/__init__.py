"""The progressive studies and reports."""
