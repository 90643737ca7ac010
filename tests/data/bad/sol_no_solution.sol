MeshVersionFormatted 2
Dimension 2
End
