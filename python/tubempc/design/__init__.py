"""Tube designs (room 4 of docs/layout.md): the LMI designs made at set-up and in the background.

- :mod:`.tube`: one subsystem's LMI design (cvxpy + Clarabel) and the tube's sets;
- :mod:`.library`: the controller's set-up designs and library, and the controller built from them;
- :mod:`.policy`: refinements run in a background process, offered to the C++ controller.
"""
