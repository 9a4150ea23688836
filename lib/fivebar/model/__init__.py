"""The linkage's equations of motion, built from a description.

Kinematics, the beam and motor elements, electromagnetics, the assembly, the nonlinear forces
(and their compiled kernel), the rigid-body and free-rotor models, the sampled equation of
motion of a set-up (``dynamics``) and its excitation.  Imports ``description``, ``numerics`` and
the root modules.
"""
