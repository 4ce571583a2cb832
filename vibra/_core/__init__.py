"""The package's own infrastructure, below every stage (issue 43: folders that show the stages):

- `vibra._core.validate`: input checks, one message style (the input named, what was expected);
- `vibra._core.filesystem`: the one writing rule (atomic writes, output folders vibra owns);
- `vibra._core.frozen`: frozen results with read-only arrays, short reprs;
- `vibra._core.lapack`: the LAPACK routines scipy does not wrap;
- `vibra._core.text`: counted nouns in messages (`counted(1, "atom")` -> "1 atom").

Private: nothing here is public API; the results' protocol is `vibra._results`.
"""
