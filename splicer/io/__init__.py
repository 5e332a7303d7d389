"""Reading and writing: BVH (and FBX through Blender), marker trajectories, the constraints file, limits, atomic output."""
