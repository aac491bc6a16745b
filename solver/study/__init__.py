"""Studies of operating points: one coupled run until periodic (simulation), its results and plots
(results, io), many runs across MPI ranks (batch), sweep files (sweep) and the summary dataset.
"""
