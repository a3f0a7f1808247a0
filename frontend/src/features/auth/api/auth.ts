import { apiPost } from '@/lib/api-client';

export type Session = 'unknown' | 'open' | 'signed-in' | 'signed-out';

/**
 * The brain says in /api/ui/config whether it has a login (so a dev brain without one sees no
 * failed request); with a login, 401 from /api/ui/config or /api/auth/me means signed out.
 */
export async function checkSession(): Promise<Session> {
  const config = await fetch('/api/ui/config', { credentials: 'same-origin' });
  if (config.status === 401) return 'signed-out';
  if (!config.ok || !((await config.json()) as { auth?: boolean }).auth) return 'open';
  const response = await fetch('/api/auth/me', { credentials: 'same-origin' });
  if (response.status === 401) return 'signed-out';
  if (response.status === 404) return 'open';
  return response.ok ? 'signed-in' : 'open';
}

export async function login(username: string, password: string): Promise<void> {
  await apiPost('/api/auth/login', { username, password });
}

export async function logout(): Promise<void> {
  await apiPost('/api/auth/logout', {});
}
