"""Ground tuning of filter-bank parameters on post-processed measurement sets: the genetic
algorithm of Chaer et al. 1997 §VII–VIII (``ga``) and EM with IRLS for the hierarchical gating
network of Chaer et al. 1998 §IV (``em_irls``). Both re-process measurements through the flight
software's own filter and gating code (``linear_bank``)."""
