"""What the book asks of the model.

Steady states and what the linkage does at a speed (``steady``, ``branches``), transient and
quasi-static responses (``response``), speed sweeps, resonance tables and Campbell data, modes
along the cycle, the multiple scales on the linkage, Figure 6, the independent multibody model,
and control of the motors (``control``).  Imports ``model``, ``description``, ``numerics`` and
the root modules.
"""
