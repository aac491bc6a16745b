"""Planar multibody dynamics: bodies and joints (multibody), time integration (integrate), cylinder
gas pressure (gas), the crank-rod-piston engine built from a case (engine) and the clearance-joint
laws of the small end (joint), which may use the film.
"""
