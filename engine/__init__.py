"""Hitpoint engine: numpy-only animation maths, BVH I/O, IK adaptation and PCA.

Never imports the app, glfw, moderngl or imgui.
"""
