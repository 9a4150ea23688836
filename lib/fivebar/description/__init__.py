"""What a linkage is and what an analysis asks.

The linkage's description (``linkage``: links, joints, sections), its parameter file
(``params``) and one analysis's set-up (``setup``: crank speed, S, motors, nonlinearity, mesh,
scheme).  Imports ``numerics`` (the schemes) and the root modules.
"""
