"""The body and its mechanics: geometry and meshes, boundary conditions, the growth tensor
C_g, the Mooney-Rivlin material, the equilibrium state, filters, and the forward model that
puts them together.  Imports the config layer and nothing above it."""
