"""Every recorded configuration still plays bit for bit the episodes it played when recorded.

The digests in ``episode_digests.json`` (see ``episode_digests.py``) are per platform;
on a platform with none recorded the comparison is skipped, saying how to record them.
"""

from __future__ import annotations

import pytest
from episode_digests import DIGEST_FILE, configurations, digest, load, platform_key

CONFIGURATIONS = configurations()


def _recorded() -> dict[str, str]:
    recorded = load()["platforms"].get(platform_key())
    if recorded is None:
        pytest.skip(f"no episode digests recorded for {platform_key()}; record them with "
                    f"`python tests/episode_digests.py --write` on the code to compare against")
    return recorded


def test_every_configuration_is_recorded():
    recorded = _recorded()
    names = {name for name, *_ in CONFIGURATIONS}
    assert set(recorded) == names, (
        f"{DIGEST_FILE.name} does not cover the configurations: missing "
        f"{sorted(names - set(recorded))}, extra {sorted(set(recorded) - names)}"
    )


@pytest.mark.parametrize(("name", "api", "opponent", "kwargs"), CONFIGURATIONS,
                         ids=[c[0] for c in CONFIGURATIONS])
def test_episodes_match_the_recorded_digest(name, api, opponent, kwargs):
    expected = _recorded().get(name)
    if expected is None:
        pytest.fail(f"{name} is not recorded in {DIGEST_FILE.name}")
    assert digest(api, opponent, kwargs) == expected, name
