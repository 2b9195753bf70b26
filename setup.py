"""Only the compiled part of the build: the cffi bindings of the C encoders (c/mkpla). Everything
else is in pyproject.toml."""

from setuptools import setup

setup(cffi_modules=["c/mkpla_cffi.py:ffi64", "c/mkpla_cffi.py:ffi32"])
