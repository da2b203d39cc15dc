#version 460
// The device BVH build, between two levels of the collapse (`collapse.comp`): the items
// the level queued become the next dispatch's work groups (the indirect arguments, spread
// over x and y as `flat_group` reads them), and the queue the level read is emptied for
// the level after.
#include "common.glsl"

layout(local_size_x = 1) in;

void main() {
    uint in_queue = pc.level & 1u;
    uint items = queue_words[1u - in_queue];
    uint groups = (items + 63u) / 64u;
    uint x = min(groups, 65535u);
    queue_words[8] = x;
    queue_words[9] = x == 0u ? 0u : (groups + x - 1u) / x;
    queue_words[10] = 1u;
    queue_words[in_queue] = 0u;
}
