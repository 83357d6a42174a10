"""The proof path: lazy rounds and their watch, parts and merges, the repairs between rounds, assembly, completion and the continuous stage. Cases I-III and the general-STL suite run nothing else."""
