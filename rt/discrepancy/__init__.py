"""The discrepancy workflow: the effects library, the virtual rig (the hidden truth) and the diagnosis (the model side)."""
