from mocapkit.cli import main

main()
