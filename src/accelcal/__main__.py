"""``python -m accelcal``: the command line, as the ``accelcal`` console script runs it."""

if __name__ == "__main__":
    from accelcal.cli import main

    main()
