import os
import sys

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy: threaded OpenBLAS is far slower here

from benchmarks.suite import main

sys.exit(main())
