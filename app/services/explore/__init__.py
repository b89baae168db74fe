"""The explorer's config and what it is turned into: the simulation, its figures, the model's
controls, the menus and the cost of a request.
"""
