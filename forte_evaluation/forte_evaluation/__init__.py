"""How good is FORTE: closed-loop grasp benchmark, slip data sets, metrics and reports."""
