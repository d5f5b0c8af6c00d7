"""Writing the result: the bake's actions, slots and NLA tracks on the character
(``bake``), and re-baking only what changed (``rebake``).

Writes only what the planner owns, found by the tag it wrote.
"""
