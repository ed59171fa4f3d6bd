"""Neural-network pieces that must run without torch (inside a stock Blender): the spectral prior,
a safetensors reader, and numpy inference operators that match torch.nn.functional."""
