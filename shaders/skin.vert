#version 330
// Linear-blend skinning into a transform-feedback buffer, once per pose: the lit pass,
// the shadow caster and the ghost then draw the skinned vertices with static.vert.
// NUM_JOINTS and WITH_NORMALS are defined by the renderer before this text.
layout(std140) uniform Bones {
    mat4 u_bones[NUM_JOINTS];    // engine.skeleton.skinning_matrices, uploaded once per pose
};
in vec3 in_pos;
in ivec4 in_joints;
in vec4 in_weights;
out vec3 out_pos;
#if WITH_NORMALS
in vec3 in_normal;
out vec3 out_normal;
#endif
void main() {
    mat4 m = in_weights.x * u_bones[in_joints.x] + in_weights.y * u_bones[in_joints.y]
           + in_weights.z * u_bones[in_joints.z] + in_weights.w * u_bones[in_joints.w];
    out_pos = (m * vec4(in_pos, 1.0)).xyz;
#if WITH_NORMALS
    out_normal = mat3(m) * in_normal;    // unnormalised, as the lit shaders normalise
#endif
}
