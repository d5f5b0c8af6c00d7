"""The command line and batches: ``blender -b ... -c footstep VERB`` and
``python -m footstep_planner VERB`` (``cli``), stdout and progress (``console``), job
lists (``batch``), baking on a Ray cluster (``ray_batch``) and the demo's review pictures
(``review``).
"""
