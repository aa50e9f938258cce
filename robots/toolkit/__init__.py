"""The localization toolkit: from laser timings to poses (docs/accuracy.md)."""
