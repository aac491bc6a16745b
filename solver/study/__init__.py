"""Studies of operating points: one coupled run until periodic (simulation: the run and its entry point;
cycles: the time loop, periodicity and checkpoints; outputs: the variables of each state, each joint
reporting its own; energy: the energy audit; film_temperature: the film's oil iterated with the cycles;
fields: ParaView), its results and plots (results, io), many runs across MPI ranks (batch), sweep files
(sweep) and the summary dataset.
"""
