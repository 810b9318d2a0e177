"""Signal processing of sampled records: whole periods, means, sine fits, phasors."""
