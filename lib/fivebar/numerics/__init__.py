"""Generic numerics, which know nothing of the linkage.

The time-integration schemes (``schemes``) and the integrator of second-order systems
(``systems``, ``newmark``, with its compiled kernels ``_kernels`` and their disk cache
``_jitcache``), Newton's method (``newton``), periodic orbits and their continuation
(``periodic``, ``continuation``), frozen modes (``eigen``), the limit of the BLAS threads
(``blas``), and the method of multiple scales on modal equations (``modal_equations``,
``multiscale``, ``response_curves``). Imports only the root modules (``errors``, ``cache``).
"""
