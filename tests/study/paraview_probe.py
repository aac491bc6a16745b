"""Open a file with ParaView's own XDMF reader and print what a user would see, as one JSON line.

Run by tests/study/test_engine_coupled.py, headless (no display needed for reading)::

    pvbatch --no-mpi paraview_probe.py FILE.xdmf TIME

Prints the reader's time steps, the data type at TIME (one grid, or a multiblock of several), its
number of points, the point arrays and their ranges at TIME.
"""

import json
import os
import sys

from paraview import servermanager
from paraview.simple import Xdmf3ReaderT

path, time = sys.argv[1], float(sys.argv[2])
if not os.path.exists(path):  # the readers only log an error and return empty data
    sys.exit(f"missing file {path}")
reader = Xdmf3ReaderT(FileName=[path])  # temporal collections as time steps
values = reader.TimestepValues  # a plain float when there is a single time step
times = [float(v) for v in values] if hasattr(values, "__len__") else [float(values)]
reader.UpdatePipeline(time)
data = servermanager.Fetch(reader)
names = sorted(reader.PointData.keys())
print(
    json.dumps(
        {
            "timesteps": times,
            "data_type": data.GetClassName(),
            "n_points": reader.GetDataInformation().GetNumberOfPoints(),
            "point_arrays": names,
            "ranges": {name: list(reader.PointData[name].GetRange()) for name in names},
        }
    )
)
