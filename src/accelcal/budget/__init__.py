"""Uncertainty budgets: the lab's standards and influence quantities through each method's model.

:mod:`accelcal.budget.gum` holds the GUM's arithmetic (inputs, rows, the
combined and expanded uncertainty, Welch-Satterthwaite); the lab file
(:mod:`accelcal.budget.lab`) and each method's measurement model (its
package's ``budget`` module, the inputs named by
:attr:`accelcal.catalog.Method.budget_inputs`) feed it through
:mod:`accelcal.budget.engine`; :mod:`accelcal.budget.mc` checks a budget by
Monte Carlo (JCGM 101). :func:`budgets` is the one call; ``accelcal
budget`` (:mod:`accelcal.cli.budget`) reads the files and prints them
(:mod:`accelcal.report.budgets`, :mod:`accelcal.budget.render`).

The package sits beside the methods (each method's ``budget`` module uses
:mod:`accelcal.budget.engine`; :func:`budgets` finds that module through the
method's descriptor).
"""


def budgets(reduction, lab=None, *, records=None, model=None, check=None) -> list:
    """The itemised GUM budget of every reported coefficient of a reduction.

    Parameters
    ----------
    reduction : accelcal.results.Reduction
    lab : accelcal.budget.lab.Lab or None
        The lab file, read by :func:`accelcal.budget.lab.load_lab`; None:
        the Type A part and the priors only.
    records : object, optional
        The data the reduction was made from, as its method reads it (a
        tumble record or its file; a dividing-head record or its file; ...).
        Without it the inputs that enter through the data are left out
        (the budgets' notes say so).
    model : accelcal.model.ErrorModel, optional
        The sensor's model, for its temperature coefficients (default: the
        reduction's models).
    check : None, "mc" or dict
        ``"mc"`` (or a dict of options): validate each budget by Monte
        Carlo; the result is the budget's ``check``. ``{"model":
        "reduction"}`` (the default): the input distributions through the
        method's reduction run again per trial
        (:func:`accelcal.budget.full.model_of`,
        :func:`accelcal.budget.mc.propagate`; the other keys ``trials``
        (None: adaptive), ``seed``, ``workers``, ``scheduler``,
        ``timeout``, ``force``, ``progress`` as it takes them; a method whose
        ``data_model`` takes ``rerun=True`` is run again in full, not
        through its first-order response);
        ``{"model": "linear"}``: through the budget's linearised model
        (:func:`accelcal.budget.mc.check`, ``trials`` and ``seed``).

    Returns
    -------
    list of accelcal.budget.gum.Budget
        One per sensor and reported coefficient (rows of
        :meth:`Reduction.rows` that are fitted; a complex one's magnitude,
        in %, and phase, in deg), in the coefficient's engineering unit, in
        the reduction's row order. Data that cannot be read again leave the
        inputs entering through them out, with a note.
    """
    import dataclasses
    import importlib
    import inspect

    from accelcal import catalog
    from accelcal.budget.engine import itemise
    from accelcal.errors import AccelcalError

    found = [m for m in catalog.METHODS if m.family == reduction.family]
    inputs = model_inputs(reduction)
    data_model, notes = None, []
    if inputs:
        module = importlib.import_module(f"{found[0].package}.budget")
        try:
            data_model = module.data_model(reduction, records)
        except (AccelcalError, OSError, ValueError) as exc:  # the data, read again, refused
            notes.append(f"the input data could not be read again ({exc})")
    if lab is None:
        from accelcal.budget.lab import empty_lab

        lab = empty_lab()
        notes.append("no lab file given: the Type A part and the priors only")
    out = itemise(reduction, lab, data_model=data_model, inputs=inputs, model=model,
                  notes=notes)
    if not check:
        return out
    options = dict(check) if isinstance(check, dict) else {}
    if options.pop("model", "reduction") == "linear":
        from accelcal.budget.mc import check as mc_check

        if options.get("trials") is None:
            options.pop("trials", None)
        return [dataclasses.replace(b, check=mc_check(b, correlation=lab.correlations,
                                                      **options)) for b in out]
    if data_model is not None and "rerun" in inspect.signature(module.data_model).parameters:
        # the reduction itself, not the first-order response the sensitivities may use
        data_model = module.data_model(reduction, records, rerun=True)
    return _checked(out, reduction, lab, data_model, model=model, options=options)


def _checked(out, reduction, lab, data_model, *, model, options) -> list:
    """``out`` with each budget's check through the full model (notes: what entered linearly)."""
    import dataclasses

    from accelcal.budget.full import model_of
    from accelcal.budget.mc import propagate

    if not out:
        return out
    study, notes = model_of(out, reduction, lab, data_model, model=model)
    checks = propagate(study, out, **options)
    done = []
    for b, c in zip(out, checks, strict=True):
        extra = [f"Monte Carlo of the full model: {n}" for n in notes]
        if c.failed:
            extra.append(f"Monte Carlo of the full model: the reduction failed in {c.failed} "
                         f"of {c.trials} trials (left out)")
        done.append(dataclasses.replace(b, check=None if c.failed == c.trials else c,
                                        notes=(*b.notes, *extra)))
    return done


def model_inputs(reduction) -> tuple:
    """The lab inputs of a reduction's measurement model.

    Its method's (:attr:`accelcal.catalog.Method.budget_inputs`), narrowed
    to the reduction's own test where the method's ``budget`` module says
    which (``inputs(reduction)``: the acceptance tests each have their own).
    """
    import importlib

    from accelcal import catalog

    found = [m for m in catalog.METHODS if m.family == reduction.family]
    if not found or not found[0].budget_inputs:
        return ()
    module = importlib.import_module(f"{found[0].package}.budget")
    narrow = getattr(module, "inputs", None)
    return tuple(narrow(reduction)) if narrow is not None else found[0].budget_inputs
