"""An example third-party pliant plugin (see docs/writing-a-plugin.md)."""
