"""Taking what a reader still holds at the stop (exodigit_nodes.logic.backlog), without ROS."""

import itertools

from exodigit_nodes.logic.backlog import take_backlog


def test_the_backlog_is_taken_until_passes_in_a_row_take_nothing():
    held = list(range(7))  # what the reader still holds; each pass of the executor takes one
    taken = []

    def spin():
        if held:
            taken.append(held.pop(0))

    assert take_backlog(spin, lambda: len(taken)) == 7
    assert taken == list(range(7))


def test_a_pass_that_handles_something_else_does_not_end_the_backlog():
    # None: a pass that handles an event, not a message (a node leaving the graph), while
    # messages still wait behind it
    passes = [0, 1, None, 2, None, None, 3, 4]
    taken = []

    def spin():
        if passes:
            message = passes.pop(0)
            if message is not None:
                taken.append(message)

    assert take_backlog(spin, lambda: len(taken)) == 5
    assert taken == [0, 1, 2, 3, 4]


def test_a_reader_that_never_runs_dry_is_left_after_the_limit():
    counter = itertools.count()
    passes = []  # a publisher still running: every pass takes something

    def spin():
        passes.append(next(counter))

    assert take_backlog(spin, lambda: len(passes), limit=0.05) == len(passes) > 0
