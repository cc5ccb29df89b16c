// Palpa, section IV: where the vertex shader finds the undeformed normal N0
// and the (nx, ny, nz, h) stream of the current vertex. Our path: two
// texture buffers indexed by the vertex id. VTK draws the mesh with its
// point ids as indices, so gl_VertexID is the vertex's index in the core.
uniform samplerBuffer palpaRestNormals;  // N0.xyz, static (uploaded once)
uniform samplerBuffer palpaStream;       // Ncorr.xyz and h (m); dirty ranges re-uploaded
vec3 palpaFetchRestNormal() { return texelFetch(palpaRestNormals, gl_VertexID).xyz; }
vec4 palpaFetchStream() { return texelFetch(palpaStream, gl_VertexID); }
