"""The package's own infrastructure, below every stage (issue 43: folders that show the stages):

- `vibra._core.validate`: input checks, one message style (the input named, what was expected);
- `vibra._core.filesystem`: the one writing rule (atomic writes, output folders vibra owns);
- `vibra._core.frozen`: frozen results with read-only arrays, short reprs;
- `vibra._core.lapack`: the LAPACK routines scipy does not wrap;
- `vibra._core.text`: counted nouns in messages (`counted(1, "atom")` -> "1 atom");
- `vibra._core.cache`: the cache folder, and values derived once per version of vibra's sources.

Private: nothing here is public API; the results' protocol is `vibra._results`.
"""

from time import time as _time

#: When this process first imported vibra (``import vibra`` imports this package first): a value
#: derived from vibra's sources is kept between processes only where none changed since
#: (`vibra._core.cache`).
IMPORTED_AT = _time()
