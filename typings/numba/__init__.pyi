# The part of numba that mocapkit uses, typed: a jitted function keeps the signature of the Python
# function it compiles. Everything else of numba is Any.
from collections.abc import Callable
from typing import Any, TypeVar, overload

_F = TypeVar("_F", bound=Callable[..., Any])

@overload
def njit(func: _F, /) -> _F: ...
@overload
def njit(*, cache: bool = ..., inline: str = ..., nogil: bool = ..., parallel: bool = ..., fastmath: bool = ...,
         **options: Any) -> Callable[[_F], _F]: ...
def prange(*args: int) -> range: ...
def __getattr__(name: str) -> Any: ...
