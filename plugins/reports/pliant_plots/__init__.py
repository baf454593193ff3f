"""Report figures for pipeline runs (matplotlib, imported only when a report is drawn)."""
