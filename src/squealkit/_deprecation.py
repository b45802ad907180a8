"""Renamed keyword arguments: the old name keeps working, with a DeprecationWarning naming the new one.

One decorator for every rename that follows the naming conventions (docs, "Conventions"), so a
rename costs one line and no caller breaks at once::

    @renamed_kwargs(freq_lower="highpass_freq")
    def response_envelope(ds, var, *, highpass_freq=1000.0): ...
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

__all__ = ["renamed_kwargs"]

F = TypeVar("F", bound=Callable[..., Any])


def renamed_kwargs(**renames: str) -> Callable[[F], F]:
    """Accept each old keyword (key) for its new name (value), warning that it is deprecated.

    Parameters
    ----------
    **renames : str
        ``old_name="new_name"`` for each renamed keyword argument.

    Returns
    -------
    callable
        A decorator. The decorated function gets the new name; passing the old one warns with a
        :class:`DeprecationWarning` (attributed to the caller), passing both is a ``TypeError``.

    Examples
    --------
    >>> import warnings
    >>> @renamed_kwargs(freq_lower="highpass_freq")
    ... def f(*, highpass_freq=1.0):
    ...     return highpass_freq
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     f(freq_lower=2.0), str(w[0].message)
    (2.0, 'f(freq_lower=...) is deprecated; use highpass_freq=... (same meaning).')
    """

    def decorate(func: F) -> F:
        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            for old, new in renames.items():
                if old in kwargs:
                    if new in kwargs:
                        raise TypeError(f"{func.__name__}() got both {old}= (deprecated) and {new}=; give {new}= only.")
                    warnings.warn(f"{func.__name__}({old}=...) is deprecated; use {new}=... (same meaning).",
                                  DeprecationWarning, stacklevel=2)
                    kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        wrapper.__renamed_kwargs__ = dict(renames)  # type: ignore[attr-defined]
        return wrapper  # type: ignore[return-value]

    return decorate
