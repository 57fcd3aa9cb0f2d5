#version 450
// Lines drawn over the map in the viewer (trajectory, keyframe frusta):
// world points projected with the viewer's pinhole camera.
layout(location = 0) in vec3 position;  // world [m]
layout(location = 1) in vec3 color;
layout(push_constant) uniform Push {
  mat4 clip_from_world;
} pc;
layout(location = 0) out vec3 v_color;
void main() {
  gl_Position = pc.clip_from_world * vec4(position, 1.0);
  v_color = color;
}
