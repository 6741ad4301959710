class SymbolicModel: pass
