"""R in the paper: the node groups, the default scenes and Cycles, and each renderer's render API."""
