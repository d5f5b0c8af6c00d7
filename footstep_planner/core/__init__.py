"""The pure core: numpy/scipy only. Nothing under this package may import bpy."""
