"""The lab: studies and report generators (not part of the dpc package). Run from the repository
root: python -m lab.<topic>.<name>; each writes its section of a page in docs/reports/."""
