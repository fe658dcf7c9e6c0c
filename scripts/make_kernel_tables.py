"""Write sarcli/formers/ffbp/kernel_tables.npy: ffbp's interpolation kernels and their error tables at
the oversamplings the planner uses (sarcli.formers.ffbp.model.TABLE_BETAS), so that planning
designs no kernel at run time. tests/test_ffbp_model.py checks the file against a fresh design.

    python scripts/make_kernel_tables.py
"""

from __future__ import annotations

import numpy as np

from sarcli.formers.ffbp import model as ffbp_model

if __name__ == "__main__":
    rows = ffbp_model.kernel_tables()
    tmp = ffbp_model.TABLE_PATH.with_suffix(".tmp.npy")
    np.save(tmp, rows)
    tmp.replace(ffbp_model.TABLE_PATH)
    print(f"{ffbp_model.TABLE_PATH}: {rows.shape[0]} oversamplings, {rows.nbytes / 1024:.0f} KiB")
