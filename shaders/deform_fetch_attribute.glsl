// Palpa, section IV: where the vertex shader finds the undeformed normal N0
// and the (nx, ny, nz, h) stream of the current vertex. VTK's own path (for
// comparison): two vertex attributes that VTK uploads as whole buffers.
in vec3 palpaRestNormalAttr;  // N0.xyz
in vec4 palpaStreamAttr;      // Ncorr.xyz and h (m)
vec3 palpaFetchRestNormal() { return palpaRestNormalAttr; }
vec4 palpaFetchStream() { return palpaStreamAttr; }
