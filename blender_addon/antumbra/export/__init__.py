"""Blender's evaluated scene as the daemon's input."""
