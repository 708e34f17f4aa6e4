"""A barrier between CPU launches running at once on several OS threads (the chain kernel's windows).

Warp's CPU atomics are plain loads and stores (a CPU launch runs on one thread), so the barrier is a native snippet
with the compiler's ``__atomic`` builtins: the last of ``parties`` to arrive resets the count and advances the
generation (release); the others spin until the generation moves (acquire), so every write before the barrier is
seen after it. A party that waits longer than ``limit`` spins sets the abort flag and returns False, and so does
every party that sees the flag: a launch whose partner is not running (more threads than free cores: a spinning
party would then hold the core its partner needs) or never came ends instead of hanging, and the host reads the flag
(``state[2]``). CPU kernels only: the snippet is plain C++ (Warp's CPU compiler takes no inline assembly).
"""

import warp as wp

BARRIER_SPIN_LIMIT = 1 << 16
"""Spins before a waiting party gives up (one spin is a load and a pause, 20–40 ns: 1–3 ms). A running partner
arrives within microseconds; one that shares its core with other work waits for its time slice, and the
windows are better given up then: every exchange would wait milliseconds."""

FIRST_WAIT_FACTOR = 64
"""The first wait of a launch may last this many times longer: it also covers the start of the other threads."""

_BARRIER = r"""
unsigned int* count = &state[0];
unsigned int* generation = &state[1];
unsigned int* aborted = &state[2];
unsigned int g = __atomic_load_n(generation, __ATOMIC_ACQUIRE);
if (__atomic_add_fetch(count, 1u, __ATOMIC_ACQ_REL) == (unsigned int)parties) {
    __atomic_store_n(count, 0u, __ATOMIC_RELAXED);
    __atomic_store_n(generation, g + 1u, __ATOMIC_RELEASE);
    return true;
}
long long spins = 0;
while (__atomic_load_n(generation, __ATOMIC_ACQUIRE) == g) {
    if (__atomic_load_n(aborted, __ATOMIC_ACQUIRE) != 0u) return false;
    if (++spins > limit) { __atomic_store_n(aborted, 1u, __ATOMIC_RELEASE); return false; }
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}
return true;
"""


@wp.func_native(_BARRIER)
def barrier(state: wp.array(dtype=wp.uint32), parties: int, limit: wp.int64) -> bool:
    """Wait until ``parties`` launches have called this on ``state`` (count, generation, abort flag; zeroed once
    before first use); False if the wait was aborted."""
    ...
