"""sse.py -- a Server-Sent Events stream, as saved by curl -N, read into its
events: one dict a blank-line-ended block, field name to value ("event",
"data", "retry"), comments and the unfinished tail left out.  Imported by
the test scripts' Python (PYTHONPATH=$SSE_LIB)."""


def events(path):
    out, cur = [], {}
    for line in open(path):
        line = line.rstrip("\n")
        if not line:
            if cur:
                out.append(cur)
                cur = {}
            continue
        k, _, v = line.partition(": ")
        cur[k] = v
    return out
