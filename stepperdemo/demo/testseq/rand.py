"""The C library ``rand()`` of the target, seeded with ``srand()``.

AVR (avr-libc): the Park-Miller "minimal standard" generator x' = 16807·x mod (2^31-1)
computed with Schrage's method, RAND_MAX = 0x7FFF.  Other targets (newlib): the
64-bit linear congruential generator of newlib, RAND_MAX = 0x7FFFFFFF.
"""

from __future__ import annotations


class AvrRand:
    RAND_MAX = 0x7FFF

    def __init__(self, seed: int) -> None:
        self.state = seed & 0xFFFFFFFF

    def rand(self) -> int:
        x = self.state
        if x == 0:
            x = 123459876
        if x & 0x80000000:
            x -= 0x100000000
        hi, lo = int(x / 127773), x - int(x / 127773) * 127773
        x = 16807 * lo - 2836 * hi
        if x < 0:
            x += 0x7FFFFFFF
        self.state = x & 0xFFFFFFFF
        return x % (self.RAND_MAX + 1)


class NewlibRand:
    RAND_MAX = 0x7FFFFFFF

    def __init__(self, seed: int) -> None:
        self.state = seed & 0xFFFFFFFFFFFFFFFF

    def rand(self) -> int:
        self.state = (self.state * 6364136223846793005 + 1) & 0xFFFFFFFFFFFFFFFF
        return (self.state >> 32) & 0x7FFFFFFF


def make_rand(profile_name: str, seed: int):
    if profile_name.startswith("atmega"):
        return AvrRand(seed)
    return NewlibRand(seed)
