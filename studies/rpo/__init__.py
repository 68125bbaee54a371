"""Exact relative periodic orbits of the FE tube's explicit scheme: u(θ, t + T) = u(θ − s, t).

``orbit`` (the time-T map on the census's batched stepper, the rotation by s, the residual
and its phase conditions), ``newton`` (Newton–Krylov with a hookstep), ``floquet`` (the
leading multipliers of the orbit), ``certificate`` (``rpo_certificate``: what the census and
``stickslip rpo`` report). Theory: docs/theory/rpo.md.
"""
