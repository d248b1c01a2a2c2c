"""The commands about one finger.

Its states (``states``), its motion under a pressure profile (``simulate``), a walker leg's cycle
(``simulate-leg``), its snap pressures (``snap``), its reset maps (``reset-maps``), and the
gripper closing on an object (``grasp``, ``sort``).
"""
