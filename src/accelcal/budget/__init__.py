"""Uncertainty budgets: the lab's standards and influence quantities through each method's model.

:mod:`accelcal.budget.gum` holds the GUM's arithmetic (inputs, rows, the
combined and expanded uncertainty, Welch-Satterthwaite); the lab file and
each method's measurement model feed it.
"""
