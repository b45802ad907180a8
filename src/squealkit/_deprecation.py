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

__all__ = ["keyword_only", "renamed_kwargs"]

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


def keyword_only(*names: str, why: str = "") -> Callable[[F], F]:
    """Make the parameters ``names`` keyword-only, still accepting them by position for one release.

    The decorated function declares ``names`` after ``*``; a call that passes them by position
    still works, with a :class:`DeprecationWarning` naming the keyword (attributed to the caller).

    Parameters
    ----------
    *names : str
        The parameters, in their former positional order, that follow the positional ones.
    why : str
        Why the keyword matters, added to the warning (e.g. what a positional value is mistaken for).

    Returns
    -------
    callable
        A decorator; the function gets ``__keyword_only__ = names``.

    Examples
    --------
    >>> import warnings
    >>> @keyword_only("tan_theta")
    ... def f(mu, *, tan_theta=0.0):
    ...     return mu + tan_theta
    >>> with warnings.catch_warnings(record=True) as w:
    ...     warnings.simplefilter("always")
    ...     f(0.4, 0.1), str(w[0].message)
    (0.5, 'f(..., tan_theta) by position is deprecated; use tan_theta=... (same meaning).')
    """

    def decorate(func: F) -> F:
        import inspect

        params = inspect.signature(func).parameters.values()
        n_positional = sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)
        if any(p.kind is p.VAR_POSITIONAL for p in params):
            raise TypeError(f"{func.__name__} takes *args: keyword_only cannot tell its positions apart.")
        keyword = {p.name for p in params if p.kind is p.KEYWORD_ONLY}
        if not set(names) <= keyword:
            raise TypeError(f"{func.__name__}: declare {', '.join(names)} after '*' (keyword-only).")

        @functools.wraps(func)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            if len(args) > n_positional:
                extra = args[n_positional:]
                if len(extra) > len(names):
                    raise TypeError(f"{func.__name__}() takes at most {n_positional + len(names)} positional "
                                    f"arguments ({len(args)} given).")
                for name, value in zip(names, extra, strict=False):
                    if name in kwargs:
                        raise TypeError(f"{func.__name__}() got {name} both by position and as {name}=.")
                    warnings.warn(f"{func.__name__}(..., {name}) by position is deprecated; use {name}=... "
                                  f"(same meaning{'; ' + why if why else ''}).", DeprecationWarning, stacklevel=2)
                    kwargs[name] = value
                args = args[:n_positional]
            return func(*args, **kwargs)

        wrapper.__keyword_only__ = tuple(names)  # type: ignore[attr-defined]
        return wrapper  # type: ignore[return-value]

    return decorate
