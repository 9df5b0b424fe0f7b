"""The symbolic core: the frozen values every later stage reads, and the passes over them.

A derivation (:mod:`mbgen.derivation`) ends in these values; optimising and
rendering code (:mod:`mbgen.codegen`), the lambdified reference
(:mod:`mbgen.runtime.lambdified`) and the checks read them and never change them.

:mod:`~mbgen.symbolic.equations`
    :class:`~mbgen.symbolic.equations.Equations`: ``M u' = F``, ``q' = G`` and
    the extras (energies, points, joint reactions, constraints, a recursion's
    program), validated on construction; its notebook summary.
:mod:`~mbgen.symbolic.layout`
    :class:`~mbgen.symbolic.layout.Layout`: the order of states, parameters and
    inputs of every array that crosses a boundary.
:mod:`~mbgen.symbolic.program`
    :class:`~mbgen.symbolic.program.Program`: named intermediates of a
    recursive derivation, and forward-mode derivatives through them.
:mod:`~mbgen.symbolic.graph`
    The passes over the expression graph: walks, substitution, operation
    counts, conversion to and from symengine, differentiation, naming shared
    nodes.
:mod:`~mbgen.symbolic.build`
    Sums and products built as sympy builds them, without its evaluation where nothing
    combines or a number is distributed over a sum (the derivation's and baking's nodes),
    one node per value inside :func:`~mbgen.symbolic.build.interned`.
:mod:`~mbgen.symbolic.availability`
    Which outputs a set of equations can give (and the error when it cannot),
    and what each sensitivity output differentiates by.
:mod:`~mbgen.symbolic.pairs`
    :class:`~mbgen.symbolic.pairs.ChainPairs`: a chain's ancestor–descendant
    products of the analytic Jacobian as per-body vectors (``Equations.pairs``).

Derived expressions share subexpressions: a deep rotation chain is a small
graph but an exponentially large tree.  Every pass here visits each distinct
node once (:func:`~mbgen.symbolic.graph.postorder_unique`,
:func:`~mbgen.symbolic.graph.walk_unique`) and memoises by node; none recurses
through the tree as sympy's own ``xreplace``, ``free_symbols`` or
``sympify`` do.

How to add a pass over the expression graph
-------------------------------------------
1. ``mbgen/symbolic/graph.py``: a function that loops over
   ``postorder_unique(exprs)`` (children first) or ``walk_unique(exprs)`` and
   keeps one result per node in a dict, as :func:`~mbgen.symbolic.graph.xreplace_dag`
   does; take an optional ``memo`` when callers pass several lists that share nodes.
2. Never call a sympy method that walks the tree on a derived expression
   (``xreplace``, ``subs``, ``free_symbols``, ``count_ops``, ``sympify`` of a
   sympy tree into symengine); a pass through a program goes through its
   assignments once (:meth:`~mbgen.symbolic.program.Program.inline`).
3. ``tests/symbolic/test_graph.py``: call the pass in ``test_passes_are_linear_in_the_graph``
   on the reproducer ``nested(N, q, c)`` (about ``2**N`` tree nodes, ``3 N``
   graph nodes, ``N = 30``): a tree walk never returns there.
"""
