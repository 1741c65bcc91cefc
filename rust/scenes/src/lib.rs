//! Built-in scenes and file import.
