from ghserver.cli import main

raise SystemExit(main())
