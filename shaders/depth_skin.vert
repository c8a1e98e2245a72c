#version 330
uniform mat4 u_view_proj;
uniform mat4 u_bones[32];
in vec3 in_pos;
in ivec4 in_joints;
in vec4 in_weights;
void main() {
    mat4 m = u_bones[in_joints.x] * in_weights.x + u_bones[in_joints.y] * in_weights.y
           + u_bones[in_joints.z] * in_weights.z + u_bones[in_joints.w] * in_weights.w;
    gl_Position = u_view_proj * (m * vec4(in_pos, 1.0));
}
