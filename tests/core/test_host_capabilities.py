"""What a host gives its components besides a clock: typed settings, and capabilities found by type."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import pytest

from aiogenomix.components.core import Component, ComponentHost, HostSettings, ManualClock
from aiogenomix.components.core.runtime import NoCapability


@dataclasses.dataclass(frozen=True)
class Lamp:
    """A capability: something that lights the room."""

    brightness: Callable[[], float]


class Bulb(Component, name="bulb"):
    """Provides a Lamp while it is loaded."""

    level = 1.0

    async def on_start(self) -> None:
        self.provide(Lamp, Lamp(lambda: self.level))


class Camera(Component, name="camera"):
    """Finds the Lamp by type, whoever provides it."""

    def exposure(self) -> float:
        lamp = self.host.find(Lamp)
        return 1.0 / lamp.brightness() if lamp is not None else 0.0


async def test_a_capability_is_found_by_type_and_goes_with_its_provider() -> None:
    async with ComponentHost(clock=ManualClock(), factories={"bulb": Bulb, "camera": Camera}) as host:
        camera = await host.load("camera")
        assert isinstance(camera, Camera) and camera.exposure() == 0.0
        with pytest.raises(NoCapability, match="no component of this host provides a Lamp"):
            host.require(Lamp)
        first = await host.load("bulb")
        second = await host.load("bulb", ["-i", "spot"])
        assert isinstance(second, Bulb)
        second.level = 4.0
        assert camera.exposure() == 0.25 and host.require(Lamp).brightness() == 4.0  # the offer made last
        await host.unload("spot")
        assert camera.exposure() == 1.0  # the one before it again
        await host.unload(first.instance)
        assert host.find(Lamp) is None


async def test_a_capability_must_be_what_it_says() -> None:
    async with ComponentHost(clock=ManualClock(), factories={}) as host:
        with pytest.raises(TypeError, match="x provides a float as a Lamp"):
            host.provide(Lamp, 1.0, by="x")  # type: ignore[arg-type]


class Broken(Component, name="broken"):
    async def on_start(self) -> None:
        self.provide(Lamp, Lamp(lambda: 1.0))
        raise RuntimeError("no bulb")


async def test_what_a_component_offered_before_failing_to_start_is_withdrawn() -> None:
    async with ComponentHost(clock=ManualClock(), factories={"broken": Broken}) as host:
        with pytest.raises(RuntimeError):
            await host.load("broken")
        assert host.find(Lamp) is None


def test_settings_are_typed_with_one_default_each() -> None:
    assert ComponentHost().settings == HostSettings()
    with pytest.raises(TypeError, match="settings are a HostSettings, not dict"):
        ComponentHost(settings={"can": "virtual"})  # type: ignore[arg-type]
    with pytest.raises(dataclasses.FrozenInstanceError):
        HostSettings().can = "socketcan:can0"  # type: ignore[misc]
    with pytest.raises(ValueError, match="can_timeout"):
        HostSettings(can_timeout=0)
    assert HostSettings(audio_files=["/srv"]).audio_files == ("/srv",)  # type: ignore[arg-type]


@dataclasses.dataclass(frozen=True)
class BulbSettings:
    watts: float = 60.0


def test_the_settings_of_other_packages_are_found_by_class() -> None:
    assert HostSettings().of(BulbSettings) == BulbSettings()  # its defaults
    assert HostSettings(extra=(BulbSettings(watts=100.0),)).of(BulbSettings).watts == 100.0


async def test_a_shared_resource_is_one_per_host_and_of_its_class() -> None:
    async with ComponentHost(clock=ManualClock(), factories={}) as host:
        made = host.shared(BulbSettings, BulbSettings)
        assert host.shared(BulbSettings, lambda: BulbSettings(1.0)) is made
        with pytest.raises(TypeError, match="the shared Lamp was made as a float"):
            host.shared(Lamp, lambda: 1.0)  # type: ignore[arg-type, return-value]
