#version 460
// The shader clock against the GPU's timestamps (src/gpu/clock_probe.rs): one invocation
// runs a chain of dependent fmas between two reads of its subgroup's clock. Cycles counted
// here over nanoseconds timed around the dispatch = the clock the shaders ran at. Compiled
// by glslang: naga has no shader clock.
#extension GL_ARB_shader_clock : require

layout(local_size_x = 1, local_size_y = 1, local_size_z = 1) in;

layout(push_constant) uniform Probe {
    uint iterations;
    float a;   // runtime values, so that the chain cannot be folded at compile time
    float b;
} probe;

layout(std430, set = 0, binding = 0) buffer Result {
    uvec2 cycles;  // low, high 32 bits
    float sink;    // the chain's value, stored so that it is computed
} result;

void main() {
    uvec2 start = clock2x32ARB();
    float x = probe.b;
    for (uint i = 0u; i < probe.iterations; i++) {
        x = fma(x, probe.a, probe.b);
    }
    result.sink = x;
    uvec2 end = clock2x32ARB();
    uint low = end.x - start.x;
    uint borrow = end.x < start.x ? 1u : 0u;
    result.cycles = uvec2(low, end.y - start.y - borrow);
}
