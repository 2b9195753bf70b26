"""The adversarial trial of issue 10 as reusable parts.

- :mod:`tests.trial.seeds`: the seed files of every reader format (tests/data excerpts and files
  generated from them: C3D, glTF/glb, points CSV) and the commands run on each;
- :mod:`tests.trial.mutators`: byte- and token-level mutations, truncation, header inflation;
- :mod:`tests.trial.generators`: deep hierarchies (BVH chains, ASF bone chains), huge claims;
- :mod:`tests.trial.runner`: one CLI run in a forked child (or a subprocess) with a timeout and an
  address-space limit, and the classification of what happened (ok, clean error, crash, hang...);
- :mod:`tests.trial.oracle`: the checks that need more than the exit code (strict JSON, written files
  read back, input hashes, devices/pipes/symlinks kept, the differential "wrong but silent" check);
- :mod:`tests.trial.cases`: the case generators per category used by ``tools/trial.py`` (hostile SQL,
  batch manifests, glTF buffer URIs and sensor names that are paths included).

The default test suite uses a few cases of each category (``tests/test_trial_*.py``); ``make fuzz``
runs thousands.
"""
