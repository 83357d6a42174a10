"""What several test modules share: dynamics tables, mission builders, paths and solving helpers.

Test modules import from here, never from one another.
"""
