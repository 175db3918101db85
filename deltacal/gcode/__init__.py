"""G-code programs rewritten for a controller: a streaming reader with the program's modal state.

* :mod:`.rewriter`: the program read line by line, every move's points corrected, the rest kept.
* :mod:`.path`: a move's intended path (lines and XY arcs) cut into the points sent.
* :mod:`.batch`: a chunk of output, its points corrected once per chunk.
"""
