"""Hysteresis Explorer application layer: command line, REST API, viser GUI, figures."""
