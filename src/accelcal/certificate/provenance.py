"""Whether a certificate's record files are the records of a store, and its chain holds.

A certificate is issued from record files. With ``--db`` each file is looked
up in the store by its content hash (the SHA-256 of its JSON: the store's
``uid`` of the record, :func:`accelcal.store.rows.calibration_row`) and the
store's hash chain is verified (:meth:`accelcal.store.Store.verify`): every
stored record against its journal entry, every link of the chain, and the
database's own integrity check. A file found in a verified store is the
record stored there, unchanged since; the certificate's ``records_chain``
says so, or names what failed.
"""

from dataclasses import dataclass


@dataclass(frozen=True)
class Provenance:
    """What the store says of a certificate's records.

    Attributes
    ----------
    statement : str
        The certificate's ``records_chain``: ``verified in store X (N records,
        chain intact)`` with the stored ids, or ``NOT verified ...`` and why.
    verified : bool
        Every record file found in the store, and its chain intact.
    """

    statement: str
    verified: bool


def store_provenance(records, names, db) -> Provenance:
    """Look the records up in the store ``db`` and verify its chain.

    Parameters
    ----------
    records : sequence of CalibrationRecord
        The certificate's records, as loaded from their files.
    names : sequence of str
        Their files, as messages show them.
    db : str or path-like or None
        The store (``--db``; None: ``ACCELCAL_DB``, else the default store).

    Returns
    -------
    Provenance
    """
    from accelcal.store import Store

    with Store(db, readonly=True) as store:
        where = store.shown
        ids = store.stored_ids(records)
        chain = store.verify()
    n = f"{chain.records} record{'s' * (chain.records != 1)}"
    missing = [(name, r.serial) for name, r, i in zip(names, records, ids, strict=True)
               if i is None]
    if missing:
        shown = ", ".join(f"{name} (serial {serial})" for name, serial in missing)
        return Provenance(f"NOT verified: not found in store {where} ({n}): {shown}", False)
    if not chain.verified:
        return Provenance(f"NOT verified: store {where}: {chain.status_line()}", False)
    stored = ", ".join(str(i) for i in ids)
    return Provenance(f"verified in store {where} ({n}, chain intact; "
                      f"record{'s' * (len(ids) != 1)} {stored})", True)
