// Palpa, section IV: per-vertex deformation inside VTK's vertex shader.
// Inserted after //VTK::Normal::Dec. VTK's attribute vertexMC holds the
// undeformed position P0 in the VBO's shifted and scaled coordinates
// ((P0 - shift) * scale per axis); normalMC (when VTK lights the surface)
// the undeformed normal N0. From here on both names mean the deformed
// values, so every later use by VTK (position, lighting, clipping,
// picking) sees the deformed surface.
uniform vec3 palpaPositionScale;  // the VBO's per-axis scale; h N0 is scaled the same way

vec4 palpaDeformedVertexMC;
void palpaDeformPosition(vec4 stream) {
  // eq. (2): P = P0 + h N0
  palpaDeformedVertexMC = vec4(vertexMC.xyz + stream.w * (palpaFetchRestNormal() * palpaPositionScale), 1.0);
}
#define vertexMC palpaDeformedVertexMC

#ifdef PALPA_DEFORM_NORMAL
vec3 palpaDeformedNormalMC;
void palpaDeformNormal(vec4 stream) {
  // eq. (3): N = normalize(N0 + sum Ni)
  palpaDeformedNormalMC = normalize(normalMC + stream.xyz);
}
#define normalMC palpaDeformedNormalMC
#endif
