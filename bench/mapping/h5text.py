"""Numbers of an HDF5 dataset or attribute, read through h5dump (hdf5-tools), for the bench
scripts that must run where h5py is not installed (Debian's python3 without python3-h5py)."""
import re
import subprocess


def h5dump(path, dataset, attribute=False):
    """The values of `dataset` (or of the attribute at that path) in `path`, flattened, as floats.
    Raises subprocess.CalledProcessError when h5dump cannot read it (missing dataset)."""
    out = subprocess.run(["h5dump", "-a" if attribute else "-d", dataset, path], capture_output=True, text=True,
                         check=True).stdout
    values = []
    for line in out.splitlines():
        m = re.match(r"\s*\(([\d,]+)\):\s*(.*)", line)
        if m and '"' not in m.group(2):
            values += [float(v) for v in m.group(2).rstrip(",").split(",") if v.strip()]
    return values
