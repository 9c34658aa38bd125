"""What a run writes: JSON, history.csv, fields.xdmf (files.py) and figures (plotting.py)."""
