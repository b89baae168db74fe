"""REST routers of the explorer, one module per resource."""
