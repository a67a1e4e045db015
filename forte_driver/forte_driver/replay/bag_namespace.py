"""The FORTE topics of a bag, in the namespace of the graph that recorded them.

A graph started with ``namespace:=right`` records ``/right/tactile/state``,
``/right/sim/ground_truth``, ... (:func:`forte_bringup.graph.recorder_topics`); a graph in
the root namespace ``/tactile/state``, ... The offline tools (:mod:`forte_bringup.report`,
:mod:`forte_evaluation.ros.slip_bags`) read a bag through :func:`read_namespaced`: given a
namespace they take its topics; without one they detect it — the namespace whose topics the
bag holds, or, when it holds those of several, a :class:`ValueError` that lists them and asks
for ``--namespace``.

Namespaces are absolute (``'/right'``) and ``''`` is the root namespace (printed ``/``), as
:func:`forte_ros.contract.graph_namespace` returns them.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path

from forte_ros.contract import graph_namespace

__all__ = ['choose_namespace', 'namespace_label', 'read_namespaced', 'split_topic']


def namespace_label(namespace: str) -> str:
    """``namespace`` as printed: ``/`` for the root namespace, else itself."""
    return namespace or '/'


def split_topic(topic: str, names: Sequence[str]) -> tuple[str, str] | None:
    """The namespace and the relative name of a bag topic, if it is one of ``names``.

    Parameters
    ----------
    topic : str
        Absolute topic name as recorded, e.g. ``/right/tactile/state``.
    names : sequence of str
        Relative topic names the caller reads, e.g. ``('tactile/state', ...)``.

    Returns
    -------
    tuple of (str, str) or None
        ``('/right', 'tactile/state')``, ``('', 'tactile/state')`` for the root namespace;
        None when the topic is none of ``names`` in a valid namespace.
    """
    for name in names:
        if not topic.endswith('/' + name):
            continue
        namespace = topic[:-len(name) - 1]
        try:
            if graph_namespace(namespace) == namespace:
                return namespace, name
        except ValueError:
            continue
    return None


def choose_namespace(found: Iterable[str], requested: str | None, bag: str | Path) -> str:
    """The namespace to read: the one asked for, or the only one the bag holds.

    Parameters
    ----------
    found : iterable of str
        Namespaces holding at least one of the caller's topics.
    requested : str or None
        The ``--namespace`` given (``right``, ``/right``, ``/`` or ``''`` for the root),
        None to detect.
    bag : str or Path
        The bag (for the messages).

    Returns
    -------
    str
        Absolute namespace, '' for the root; the root when nothing is found and nothing
        was asked for (the caller then reports what is missing).

    Raises
    ------
    ValueError
        If ``requested`` is not a valid namespace, or the bag holds the caller's topics in
        other namespaces only, or (detecting) in several namespaces.
    """
    found = sorted(set(found))
    listed = ', '.join(namespace_label(namespace) for namespace in found)
    if requested is not None:
        namespace = graph_namespace(requested)
        if found and namespace not in found:
            raise ValueError(f'{bag}: no FORTE topics in namespace '
                             f'{namespace_label(namespace)}; the bag has them in: {listed}')
        return namespace
    if len(found) > 1:
        raise ValueError(f'{bag}: the bag holds the FORTE topics of several namespaces '
                         f'({listed}); choose one with --namespace, e.g. --namespace '
                         f'{namespace_label(found[-1])}')
    return found[0] if found else ''


def read_namespaced(bag: str | Path, names: Sequence[str], namespace: str | None = None
                    ) -> tuple[str, dict[str, list]]:
    """The messages of ``names`` in one namespace of a bag, in one pass over the bag.

    Parameters
    ----------
    bag : str or Path
        rosbag2 folder or ``.mcap`` file.
    names : sequence of str
        Relative topic names to read (e.g. ``('tactile/state', 'sim/ground_truth')``).
    namespace : str, optional
        The namespace to read (``right``, ``/right``; ``/`` or ``''`` for the root);
        None: detect it (:func:`choose_namespace`).

    Returns
    -------
    namespace : str
        The namespace read ('' = root).
    messages : dict of str to list
        Relative name -> its serialized messages
        (:class:`forte_driver.replay.mcap_source.BagMessage`), in file order.

    Raises
    ------
    ValueError
        As :func:`choose_namespace`.
    forte_driver.replay.mcap_source.BagError
        If the bag cannot be read.
    """
    from forte_driver.replay.bags import read_bag

    by_namespace: dict[str, dict[str, list]] = {}
    for message in read_bag(bag):
        where = split_topic(message.topic, names)
        if where is not None:
            found = by_namespace.setdefault(where[0], {name: [] for name in names})
            found[where[1]].append(message)
    chosen = choose_namespace(by_namespace, namespace, bag)
    return chosen, by_namespace.get(chosen, {name: [] for name in names})
