#!/usr/bin/env python3
"""Where two images of one view differ: the image cut into N x N blocks, each block's mean
(over channels) of A divided by B's, printed as a table (top row first), with the whole
image's ratio. A bias that the image mean hides (one wall too dark, another too bright) shows
here: docs/results/h100/tail/README.md.

    python3 tools/mitsuba/region-ratios.py A.exr B.exr [N]   (N default 8)

Blocks where B's mean is below 1e-4 print as "-".
"""
import sys
sys.path.insert(0,'/work/main/tools/mitsuba')
from compare import read
import numpy as np
a=read(sys.argv[1]).mean(axis=2); b=read(sys.argv[2]).mean(axis=2)
n=int(sys.argv[3]) if len(sys.argv)>3 else 8
h,w=a.shape; bh,bw=h//n,w//n
print(f"mean ratio {a.mean()/b.mean():.4f}")
for i in range(n):
    row=[]
    for j in range(n):
        sa=a[i*bh:(i+1)*bh,j*bw:(j+1)*bw].mean(); sb=b[i*bh:(i+1)*bh,j*bw:(j+1)*bw].mean()
        row.append(f"{sa/sb:6.3f}" if sb>1e-4 else "   -  ")
    print(' '.join(row))
