"""Frames through the daemon: the one frame job (``frame_job``) and what drives it (comparisons,
trades), the spool's batches, and what a finished frame becomes (images, files, tables)."""
