"""The viser GUI of the explorer: per-client layout bound to sessions, render workers."""
