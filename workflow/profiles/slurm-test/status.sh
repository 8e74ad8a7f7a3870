#!/usr/bin/env bash
# Job status for Snakemake's cluster-generic executor from squeue alone (no accounting needed):
# success, failed or running. squeue knows a finished job for MinJobAge seconds (300 in the
# tests' slurm.conf); a job it does not know (yet) counts as running.
state=$(squeue -h --states=all -j "$1" -o %T 2>/dev/null | head -1)
case $state in
  COMPLETED) echo success ;;
  PENDING | CONFIGURING | RUNNING | COMPLETING | SUSPENDED | RESIZING | REQUEUED | "") echo running ;;
  *) echo failed ;;
esac
